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
