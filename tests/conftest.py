"""Shared fixtures: every shipped case's quick variant, run once per test session."""
from __future__ import annotations

import signal
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
