"""Shared fixtures: every shipped case's quick variant, run once per test session."""
from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import os

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run and machine (a CI run must not fail on an
# example no earlier run drew; test_hard_cases.py once met an elastic stop 1e-129 above rest
# that way): HYPOTHESIS_PROFILE=explore draws new ones, to hunt for more.
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml"))


@pytest.fixture(scope="session")
def quick_results(tmp_path_factory):
    """``quick_results(case_path) -> results folder`` of ``vibeam run CASE --quick --no-plots``
    (inline), computed on the first request and shared by the tests that read it (regression
    against the references, xarray layout, figures: tests/test_plots.py builds every figure
    from the file)."""
    from vibeam.cli import main

    done: dict = {}

    def get(path) -> Path:
        path = Path(path)
        if path not in done:
            out = tmp_path_factory.mktemp(path.stem)
            warm = Path(os.environ.get(QUICK_DIR_ENV, "/nonexistent")) / path.stem
            if (warm / "done").exists() and (warm / "out" / "results.h5").exists():
                # the warm-up's run of this case (pytest_sessionstart): the same command
                shutil.copytree(warm / "out", out, dirs_exist_ok=True)
            else:
                rc = main(["run", str(path), "--quick", "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"])
                assert rc == 0, f"vibeam run {path} --quick exited {rc}"
            done[path] = out
        return done[path]

    return get


def pytest_configure(config):
    """Ctrl-C's default disposition in this process, so the vibeam processes the interrupt tests
    start (which inherit it across exec) stop on SIGINT: a shell without job control starts a
    background command (``pytest ... &`` in a script, a CI step) with SIGINT ignored, and such a
    child ran its map to the end and exited 0 (test_map.py::test_ctrl_c_keeps_finished_lines)."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


# ----------------------------------------------------------------------------- the warm-up
#: where the warm-up leaves each shipped case's quick run (``<dir>/<stem>/out``)
QUICK_DIR_ENV = "VIBEAM_TEST_QUICK_DIR"

_WARM = """
import sys
from pathlib import Path
from vibeam.cli import main
dest = Path(sys.argv[1])
for case in sys.argv[2:]:
    d = dest / Path(case).stem
    rc = main(["run", case, "--quick", "--out", str(d / "out"), "--jobs", "1", "--quiet", "--no-plots"])
    if rc == 0:
        (d / "done").write_text("")
"""


def pytest_sessionstart(session):
    """With an empty numba cache, every xdist worker compiles the kernels it meets, and two
    workers meet the same ones at the same time: the whole suite's common kernels compiled
    twice.  The controller therefore first runs every shipped case's quick variant (the runs the
    ``quick_results`` fixture needs anyway) in two processes, the SDOF cases in one and the beam
    cases in the other, which compile disjoint kernel families into numba's shared on-disk cache;
    the workers then load them, and the fixture copies those runs instead of repeating them.

    Only for the whole suite under xdist (``pytest`` with its testpaths and ``-n``); a run that
    fails here is left to the fixture, which runs it again and reports it.
    ``VIBEAM_TEST_WARMUP=0`` turns it off."""
    config = session.config
    if hasattr(config, "workerinput") or os.environ.get("VIBEAM_TEST_WARMUP", "1") == "0":
        return
    n = getattr(config.option, "numprocesses", None)
    if not n or n == 0 or config.args_source != pytest.Config.ArgsSource.TESTPATHS:
        return
    dest = Path(tempfile.mkdtemp(prefix="vibeam-quick-"))
    import tomllib

    beam = [str(c) for c in CASES if tomllib.loads(c.read_text()).get("model", {}).get("fidelity") == "beam"]
    sdof = [str(c) for c in CASES if str(c) not in beam]
    procs = [subprocess.Popen([sys.executable, "-c", _WARM, str(dest), *group], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for group in (sdof, beam)]
    for p in procs:
        p.wait()
    os.environ[QUICK_DIR_ENV] = str(dest)
