"""Shared fixtures: every shipped case's quick variant, run once per test session."""
from __future__ import annotations

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
