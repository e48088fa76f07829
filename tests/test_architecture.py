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


# ----------------------------------------------------------------------------- the fidelity registry
def test_every_registered_fidelity_has_a_spec_and_every_spec_a_fidelity():
    from vibeam.case import MODEL_SPECS
    from vibeam.models.registry import FIDELITIES, resolve

    assert set(MODEL_SPECS) == set(FIDELITIES)
    for name, f in FIDELITIES.items():
        assert resolve(f.model).fidelity == name
        for method, path in f.methods.items():
            assert resolve(path).name == method, (name, method)
        assert set(f.modal_state_methods) <= set(f.methods)
        assert set(f.restitution_law_methods) <= set(f.methods)
        spec = MODEL_SPECS[name]
        for attr in ("build", "dofs", "check", "result_attrs", "converged_reference", "effect_model",
                     "case_update"):
            assert callable(getattr(spec, attr, None)), (name, attr)


def test_the_framework_has_no_fidelity_branches():
    """``fidelity == "beam"`` and the like: the framework asks the registry instead."""
    import re

    pat = re.compile(r"""fidelity['"\])]*\s*[!=]=\s*['"]""")
    files = sorted((ROOT / "vibeam").glob("*.py")) + [ROOT / "tests" / "references" / "make_references.py"]
    bad = [f"{p.name}:{i}: {line.strip()}" for p in files
           for i, line in enumerate(p.read_text().splitlines(), 1) if pat.search(line)]
    assert not bad, bad


def test_validating_a_case_loads_no_solver():
    """The case validator reads the registry, which is pure Python: no kernel module, no scipy."""
    import subprocess
    import sys

    code = ("import sys; from vibeam.case import load_case; load_case(sys.argv[1]); "
            "bad = sorted(m for m in sys.modules if m.startswith(('scipy.integrate', 'scipy.linalg', "
            "'scipy.optimize', 'skfem', 'vibeam.models.sdof', 'vibeam.models.beam'))); print(bad)")
    p = subprocess.run([sys.executable, "-c", code, str(ROOT / "cases" / "rig-fe-tight.toml")],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]", p.stdout


def test_make_solver_and_shooting_come_from_the_registry():
    from vibeam.models import SHOOTING, SDOF, make_solver
    from vibeam.models.registry import FIDELITIES, resolve

    m = SDOF(beta=0.01, B=1e-3, R=0.8, Delta=0.0)
    for method, path in FIDELITIES["sdof"].methods.items():
        assert type(make_solver(m, method)) is resolve(path)
    assert set(SHOOTING) == {n for n, f in FIDELITIES.items() if f.shooting}
    with pytest.raises(ValueError, match="allowed: averaging, direct, event"):
        make_solver(m, "nope")
