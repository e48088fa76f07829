"""The architecture rules of vibeam that code review alone would let slip.

* ``models/`` (the fidelities) and ``reductions/`` never import the framework (``vibeam.*``
  outside ``vibeam.models`` and ``vibeam.reductions``): the models produce plain data
  (:class:`vibeam.models.trajectory.Trajectory`) that the framework consumes.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ALLOWED = ("vibeam.models", "vibeam.reductions")


def _imports(path: Path):
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.lineno, node.module


@pytest.mark.parametrize("folder", ["models", "reductions"])
def test_models_do_not_import_the_framework(folder):
    bad = []
    for p in sorted((ROOT / folder).glob("*.py")):
        for line, mod in _imports(p):
            if (mod == "vibeam" or mod.startswith("vibeam.")) and not mod.startswith(ALLOWED):
                bad.append(f"{folder}/{p.name}:{line} imports {mod}")
    assert not bad, bad


def test_trajectory_is_the_models_class_reexported_by_the_framework():
    from vibeam.models.trajectory import Trajectory
    from vibeam.records import Trajectory as T2

    assert T2 is Trajectory and Trajectory.__module__ == "vibeam.models.trajectory"
