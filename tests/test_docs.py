"""The generated documentation is complete and up to date (issue 22: cases/README.md).

Each test can fail: a key added to the schema without a meaning, a meaning left behind for a
removed key, a case without a description, or a cases/README.md not regenerated after a change.
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
    seen, todo = set(), [schema.Case, *schema.MODEL_SPECS.values()]

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
    text = (CASES / "README.md").read_text(encoding="utf-8")
    assert text == reference.cases_readme(CASES), \
        "cases/README.md is out of date: run `python -m vibeam.case.reference`"


def test_type_descriptions():
    from typing import Annotated, Literal

    from pydantic import Field

    assert reference.describe_type(Annotated[float, Field(ge=0.0, le=1.0)]) == "number (>= 0, <= 1)"
    assert reference.describe_type(Literal["up", "down"]) == '"up" | "down"'
    assert reference.describe_type(Annotated[list[float], Field(min_length=2, max_length=2)] | None) \
        == "list of number (length 2)"
