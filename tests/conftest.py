"""Shared fixtures: every shipped case's quick variant, run once per test session."""
from __future__ import annotations

import signal
from pathlib import Path

import pytest

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
