"""The documentation is complete, up to date and true to the code.

Each test can fail: a key added to the schema without a meaning, a meaning left behind for a
removed key, a case without a description, a generated block of cases/README.md not regenerated
after a change, a README.md longer than a newcomer reads, a test named in the validation table of
tests/README.md that does not exist, or a documented results layout that does not open.
"""
from pathlib import Path

import pytest

from vibeam.case import reference

CASES = Path(__file__).resolve().parents[1] / "cases"


@pytest.mark.parametrize("heading,model,note", reference.TABLES, ids=[t[0] for t in reference.TABLES])
def test_every_key_has_unit_and_meaning(heading, model, note):
    keys = set(reference.table_keys(heading, model))
    documented = set(reference.MEANINGS[heading])
    assert keys - documented == set(), f"{heading}: keys of the schema without a meaning"
    assert documented - keys == set(), f"{heading}: meanings of keys the schema does not have"
    assert all(m for _, m in reference.MEANINGS[heading].values())


def test_every_table_of_the_schema_is_documented():
    """Every pydantic model reachable from a case (by field annotation) has a heading."""
    import typing

    from pydantic import BaseModel

    from vibeam.case import schema

    documented = {m for _, m, _ in reference.TABLES}
    # one heading ("[model] (canonical: [model.system] builder = "sdof" or "beam")") documents both
    # paper builders' [model]: the same three tables
    assert schema.SDOFSceneSpec in documented
    assert set(schema.BeamSceneSpec.model_fields) == set(schema.SDOFSceneSpec.model_fields)
    documented.add(schema.BeamSceneSpec)
    from vibeam.case.expand import SHORTHAND_FIDELITIES

    # the specs of every [model.system] builder and the shorthand tables (the key reference's models
    # of the keys a shorthand [model] may have: vibeam.case.reference.shorthand_table)
    seen, todo = set(), [schema.Case, *schema.CANONICAL_SPECS.values(),
                         *(reference.shorthand_table(f) for f in SHORTHAND_FIDELITIES)]

    def models_in(ann):
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            yield ann
        for a in typing.get_args(ann):
            yield from models_in(a)

    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        for f in m.model_fields.values():
            todo += list(models_in(f.annotation))
    missing = {m.__name__ for m in seen} - {m.__name__ for m in documented}
    assert missing == set()


def test_every_shipped_case_has_a_description():
    rows = reference.catalogue(CASES)
    assert len(rows) == len(list(CASES.glob("*.toml"))) > 20
    assert [n for n, _, d in rows if len(d) < 20] == []


def test_cases_readme_is_up_to_date():
    """The generated blocks equal what the generator writes now; the hand-written guide is there."""
    text = (CASES / "README.md").read_text(encoding="utf-8")
    assert text == reference.cases_readme(CASES, text), \
        "cases/README.md is out of date: run `python -m vibeam.case.reference`"
    outside = text
    for name in reference.BLOCKS:
        head, rest = outside.split(f"<!-- begin generated: {name} -->")
        outside = head + rest.split(f"<!-- end generated: {name} -->")[1]
    assert "## Writing a scene" in outside   # the guide is hand-written, between the two blocks
    assert text.index("generated: catalogue -->") < text.index("## Writing a scene") \
        < text.index("<!-- begin generated: keys -->")


def test_generator_rewrites_only_its_blocks():
    """Text outside the markers is kept byte for byte; a stale block is replaced; a missing or
    repeated marker is an error naming the file."""
    from vibeam.errors import InputError

    blocks = {"catalogue": "NEW CATALOGUE", "keys": "NEW KEYS"}
    text = ("# hand\n\nintro ü\n<!-- begin generated: catalogue -->\nstale\n"
            "<!-- end generated: catalogue -->\n\nguide\n  kept  \n"
            "<!-- begin generated: keys -->\n<!-- end generated: keys -->\ntail\n")
    out = reference.fill_blocks(text, blocks)
    assert out == ("# hand\n\nintro ü\n<!-- begin generated: catalogue -->\nNEW CATALOGUE\n"
                   "<!-- end generated: catalogue -->\n\nguide\n  kept  \n"
                   "<!-- begin generated: keys -->\nNEW KEYS\n<!-- end generated: keys -->\ntail\n")
    assert reference.fill_blocks(out, blocks) == out
    for bad in (text.replace("<!-- end generated: keys -->", ""),
                text + "<!-- begin generated: catalogue -->\n"):
        with pytest.raises(InputError, match="README.md"):
            reference.fill_blocks(bad, blocks)
    assert reference.fill_blocks(reference.skeleton(), blocks).count("NEW") == 2


def test_type_descriptions():
    from typing import Annotated, Literal

    from pydantic import Field

    assert reference.describe_type(Annotated[float, Field(ge=0.0, le=1.0)]) == "number (>= 0, <= 1)"
    assert reference.describe_type(Literal["up", "down"]) == '"up" | "down"'
    assert reference.describe_type(Annotated[list[float], Field(min_length=2, max_length=2)] | None) \
        == "list of number (length 2)"


def _python_blocks(text: str) -> list[str]:
    import re

    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_documented_branch_layout_opens(tmp_path, monkeypatch):
    """The continuation layout of cases/README.md opens as documented: its code block runs on a
    file written by the one branch writer (vibeam.analysis.branches.write_branches) and finds the
    branches on (branch, point) and the bifurcations in their subgroup."""
    import h5py
    import numpy as np

    from vibeam.analysis.branches import ContinuationResult, write_branches

    text = (CASES / "README.md").read_text(encoding="utf-8")
    code = [b for b in _python_blocks(text) if 'group="branches/' in b]
    assert len(code) == 1
    data = [dict(parameter=np.linspace(1.5, 2.5, n), amplitude=np.linspace(1e-3, 2e-3, n),
                 stable=np.arange(n) < 3, period=np.full(n, p, np.int64)) for n, p in ((5, 1), (3, 2))]
    bif = dict(type="period_doubling", parameter=2.28, branch=0, n=1, amplitude=1.7e-3, detail="multiplier -1")
    r = ContinuationResult(
        name="branches", fidelity="sdof", parameter="Omega", settings={},
        branches=[dict(index=i, data=d, n=int(d["period"][0]), status="range_end", message="", origin="test",
                       bifurcations=[bif] if i == 0 else []) for i, d in enumerate(data)],
        starts=[], curves=[], status="ok", message="", wall_time_s=0.0)
    out = tmp_path / "results" / "paper-fig13-continuation"
    out.mkdir(parents=True)
    with h5py.File(out / "results.h5", "w") as f:
        write_branches(f, [r])
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(code[0], ns)   # prints the bifurcation types and parameters
    assert ns["p1"].sizes["point"] == 5 and ns["br"].amplitude.dims == ("branch", "point")
    assert np.allclose(ns["p1"].parameter.values, data[0]["parameter"])
    assert list(ns["bif"].type.values) == ["period_doubling"]
    assert int(ns["bif"].bifurcation_branch[0]) == 0


def _validation_node_ids() -> list[str]:
    import re

    text = (Path(__file__).resolve().parent / "README.md").read_text(encoding="utf-8")
    section = text.split("## Validation evidence", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and "::" in line]
    assert len(rows) >= 50, "the validation table lost its rows"
    ids = []
    for row in rows:
        found = re.findall(r"`(tests/test_\w+\.py::\w+)`", row.rsplit("|", 2)[-2])
        assert found, f"a row of the validation table names no test: {row[:80]}"
        ids += found
    return ids


def test_every_test_named_in_the_validation_table_exists():
    """Each `tests/test_x.py::test_name` of tests/README.md's validation table is a test function
    defined in that file (found in its syntax tree, so a renamed or removed test fails here)."""
    import ast

    root = Path(__file__).resolve().parents[1]
    missing = []
    for node in _validation_node_ids():
        path, name = node.split("::")
        tree = ast.parse((root / path).read_text(encoding="utf-8")) if (root / path).is_file() else None
        defined = set() if tree is None else \
            {n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
        if not name.startswith("test_") or name not in defined:
            missing.append(node)
    assert missing == []


def test_readme_is_short_and_keeps_the_quick_start():
    """README.md is what a newcomer reads first: at most 300 lines, with the two quick-start
    commands unchanged (CI and users copy them) and pointers to the longer documents."""
    text = (CASES.parent / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    lines = text.splitlines()
    assert "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/vibeam run cases/paper-fig7.toml" in lines
    assert "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/python -m pytest" in lines
    for doc in ("cases/README.md", "tests/README.md"):
        assert doc in text and (CASES.parent / doc).is_file()


def test_vibeam_cases_prints_the_catalogue(capsys, tmp_path):
    from vibeam.cli import main

    assert main(["cases", str(CASES)]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = reference.catalogue(CASES)
    assert len(out) == len(rows)
    for line, (name, fid, desc) in zip(out, rows):
        assert line.startswith(name) and line.rstrip().endswith(desc) and f" {fid} " in line
    assert main(["cases", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path) in err and "no case files" in err and err.count("\n") == 1
