"""tests/mutation.py's own parts (issue 56): the mutants it makes from one parse of a module are
cosmic-ray's, the lines it counts as reached, the modules a mutant's child imports afresh."""
from __future__ import annotations

import pytest

pytest.importorskip("cosmic_ray")


def _driver():
    """tests/mutation.py, loaded from its file (``tests`` is not a package on every pytest path)."""
    import importlib.util
    import sys
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("vibeam_tests_mutation", Path(__file__).with_name("mutation.py"))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


_d = _driver()
_Mutator, _dependents, _import_lines, _statement_lines = _d._Mutator, _d._dependents, _d._import_lines, _d._statement_lines

SOURCE = '''"""A module with a site for every operator."""
import math

LIMIT = 2 ** 16


@staticmethod
def f(x: float | None, y=3) -> float:
    if x is None or y > 1 and not x < -2.5:
        return -x
    total = 0
    for k in range(y):
        if k == 2:
            continue
        total += k * 2 - 1 / 3 % 4 // 5
        if total >= 10:
            break
    try:
        return math.sqrt(total) + (x != y) - (x <= y)
    except (ValueError, TypeError):
        return True
    finally:
        pass


class C:
    size: int = 1

    def g(self, a):
        while a > 0:
            a -= 1
        return a << 1 | a >> 2 & ~a ^ +a
'''


def test_the_mutants_made_from_one_parse_are_cosmic_rays():
    """For one operator of each kind (binary, comparison, unary operators, numbers, not, and/or,
    keywords, exceptions, loops, ...), its last site counted from the one parse gives cosmic-ray's
    mutant (its visitor re-parses and counts), and one past it gives none, as cosmic-ray's (every
    operator on the four modules of issue 56: 458 of 458, by hand)."""
    from types import SimpleNamespace

    import cosmic_ray.plugins
    from cosmic_ray.mutating import mutate_code

    mu = _Mutator(SOURCE)
    used, kinds = 0, set()
    for name in sorted(cosmic_ray.plugins.operator_names(), reverse=True):
        op = cosmic_ray.plugins.get_operator(name)
        kind = name.split("/")[-1].split("_")[0]
        if op.arguments() or kind in kinds:
            continue
        n = sum(len(list(op().mutation_positions(node))) for node in mu.nodes)
        if n == 0:
            continue
        used += 1
        kinds.add(kind)
        spec = SimpleNamespace(operator_name=name, occurrence=n - 1)
        assert mu.mutated(spec) == mutate_code(SOURCE, op(), n - 1) != SOURCE, name
        assert mu.mutated(SimpleNamespace(operator_name=name, occurrence=n)) is None
        assert mutate_code(SOURCE, op(), n) is None
    assert used >= 10, kinds


def test_the_lines_a_mutant_needs_run():
    own = _statement_lines(SOURCE)
    assert own[15] == frozenset({15})                       # a simple statement: its own line
    assert own[9] == frozenset({9})                         # an if: its header, not its body
    assert own[7] == own[8] == frozenset({7, 8})            # a decorated def: decorator and header
    at_import = _import_lines(SOURCE)
    assert {1, 2, 4, 7, 8, 26, 27, 29} <= at_import and not {9, 10, 15, 30, 32} & at_import


def test_a_child_imports_afresh_the_mutated_module_and_its_importers():
    graph = {"p": set(), "p.a": set(), "p.b": {"p.a"}, "p.c": {"p.b"}, "p.d": set(), "p.q": {"p.c"},
             "p.q.x": set()}
    assert _dependents(graph, "p.a") == {"p.a", "p.b", "p.c", "p.q", "p.q.x"}
    assert _dependents(graph, "p.d") == {"p.d"}
