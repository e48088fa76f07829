"""Newton's R is held and checked by its law (issue 58: "R's range checked in one place"):
:class:`vibeam.models.contact.Restitution` refuses an R outside [0, 1] when it is made, through
:func:`vibeam.models.contact.restitution_problem`, and no other range check of an R is left in
the dynamics; the case tables call the same function for the key the user wrote
(:func:`vibeam.case.contact.check_restitution`), so no second range of R is written anywhere."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from vibeam.models.contact import Restitution, restitution_problem
from vibeam.models.builders.sdof import sdof

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("R", [-1e-300, -0.1, 1.0 + 2.0**-52, 1.5, math.nan, math.inf, -math.inf])
def test_restitution_refuses_an_R_outside_0_1(R):
    with pytest.raises(ValueError, match=r"R must lie in \[0, 1\], got"):
        Restitution(R)
    assert restitution_problem(R, "R_lower").startswith("R_lower must lie in [0, 1]")


@pytest.mark.parametrize("R", [0.0, -0.0, 1e-300, 0.5, 1.0])
def test_restitution_takes_every_R_in_0_1(R):
    assert Restitution(R).R == R and restitution_problem(R) == ""


def test_a_model_with_a_bad_R_is_refused_when_it_is_made():
    with pytest.raises(ValueError, match=r"R must lie in \[0, 1\], got 1.2"):
        sdof(beta=0.02, B=0.5, Delta=0.0, R=0.8, Delta_lower=1.0, lower_law=Restitution(float(1.2)))
    with pytest.raises(ValueError, match=r"R must lie in \[0, 1\], got -0.5"):
        sdof(beta=0.02, B=0.5, Delta=0.0, R=-0.5)


#: a range check of an R (``0 <= R <= 1``, ``not 0.0 <= x.R <= 1.0``, ...) in source text
_CHECK = re.compile(r"0(\.0)?\s*<=\s*[\w.\[\]()]*\bR(_lower)?\b[\w.\[\]()]*\s*<=\s*1(\.0)?")


def test_no_other_range_check_of_R_in_the_dynamics():
    hits = []
    for path in sorted((ROOT / "models").rglob("*.py")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#")[0]
            if _CHECK.search(code) and "``" not in code and "restitution_problem" not in code \
                    and 'else f"{name} must lie' not in code:
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert hits == [], "\n".join(hits)


def test_the_laws_table_values_are_checked_by_the_law():
    """A velocity-dependent R (paper Fig. 26) is Newton's law too: each table value in [0, 1]."""
    assert Restitution(0.8, (0.0, 1.0), (0.5, 1.0)).table_R == (0.5, 1.0)
    with pytest.raises(ValueError, match=r"R\(U-\) must lie in \[0, 1\], got 1.2"):
        Restitution(0.8, (0.0, 1.0), (0.5, 1.2))


#: a pydantic range bound written beside an R field (``R: Annotated[float, Field(ge=0.0, le=1.0)]``)
_BOUND = re.compile(r"\bR(_lower)?\b.*Field\(\s*ge\s*=\s*0(\.0)?\s*,\s*le\s*=\s*1(\.0)?\s*\)")


def test_the_case_layer_checks_R_by_the_laws_function():
    """The case layer writes no range of its own for R: its fields use
    :data:`vibeam.case.contact.RestitutionValue`, which calls :func:`restitution_problem`
    (two bounds ``Field(ge=0.0, le=1.0)`` before: ``[model.contact] R`` and
    ``[effects.restitution_law] R``).  The messages still name the key and the value."""
    from vibeam.case.schema import parse_case
    from vibeam.errors import CaseError

    hits = []
    for path in sorted((ROOT / "vibeam").rglob("*.py")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if _BOUND.search(line.split("#")[0]):
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert hits == [], "\n".join(hits)
    text = (ROOT / "cases" / "paper-fig7.toml").read_text()
    assert "\nR = 0.9\n" in text
    with pytest.raises(CaseError) as e:
        parse_case(text.replace("\nR = 0.9\n", "\nR = 1.25\n", 1), "bad.toml")
    msg = str(e.value)
    assert msg.startswith("bad.toml: 'model.R' = 1.25: R must lie in [0, 1], got 1.25") and "\n" not in msg, msg
