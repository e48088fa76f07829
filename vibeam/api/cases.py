"""Cases for the API: :func:`load_case` (a path, TOML text, a dict or a Case), the text a case came
from (:func:`case_text`, for its results file) and the run of a case a function is given."""
from __future__ import annotations

import json
import os
import tomllib
import weakref
from pathlib import Path

from pydantic import ValidationError

from vibeam.case.schema import Case, load_case as load_case_file, parse_case, validation_message
from vibeam.errors import CaseError, quote_value


def load_case(source):
    """A validated case from a file, TOML text or a dict.

    Parameters
    ----------
    source : str, Path, dict or vibeam.case.schema.Case
        A path to a case file (``.toml``); the TOML text of a case (any string with a
        newline, or one that is not an existing file); a dict with the case's tables
        (as ``tomllib`` would read them); or a Case (returned as it is).

    Returns
    -------
    vibeam.case.schema.Case
        The case; its text (for the results file) is in ``case_text(case)``.

    Raises
    ------
    vibeam.case.schema.CaseError
        If the file cannot be read (not a regular file, larger than 10 MB:
        :func:`vibeam.io.inputs.read_input_text`) or the case is invalid (one line naming the
        key, the value and what is allowed).
    TypeError
        If ``source`` is none of the above (None, a number, bytes, ...).
    """
    if isinstance(source, Case):
        return source
    if not isinstance(source, (str, os.PathLike, dict)):
        raise TypeError(f"source = {quote_value(source)}: not a case; allowed: a path to a case file (str or "
                        f"pathlib.Path), the TOML text of a case, a dict of its tables or a Case")
    if isinstance(source, dict):
        text = _toml_text(source)
        try:
            tomllib.loads(text)
        except tomllib.TOMLDecodeError:      # not writable as TOML: validate the dict as it is
            try:
                case = Case.model_validate(source)
            except ValidationError as e:
                raise CaseError(validation_message(e, "", Case)) from None
            return remember(case, "")
        return remember(parse_case(text, "<dict>"), text)
    if not isinstance(source, str) or names_a_file(source):
        case, text = load_case_file(source)
        return remember(case, text)
    return remember(parse_case(source, "<text>"), source)


def names_a_file(text: str) -> bool:
    """Is a string given to :func:`load_case` a path (rather than TOML text)?  One line that
    names something on disk (a file, a folder, a device: what is not a regular file is then
    refused as such), ends with ``.toml``, is empty, or could not be TOML (no ``=``)."""
    if "\n" in text:
        return False
    if not text.strip() or text.endswith(".toml") or "=" not in text:
        return True
    try:
        return Path(text).exists()
    except (OSError, ValueError):        # a name too long, a NUL byte: not a file
        return False


_TEXT: dict = {}


def remember(case, text: str):
    """Keep the text a case came from (for its results file) as long as the case lives."""
    _TEXT[id(case)] = text
    weakref.finalize(case, _TEXT.pop, id(case), None)
    return case


def case_text(case) -> str:
    """The TOML text a case was loaded from (by :func:`load_case`), else one written from it."""
    return _TEXT.get(id(case)) or _toml_text(case.model_dump(exclude_none=True))


def _toml_text(d: dict, prefix: str = "") -> str:
    """TOML text of a case dict (tables and arrays of tables; strings, numbers, lists)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        return repr(float(v)) if isinstance(v, float) else str(v)

    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v))
        elif v is not None:
            lines.append(f"{json.dumps(k) if not k.isidentifier() else k} = {val(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in tables:
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out += f"\n[{name}]\n" + _toml_text(v, name + ".")
        else:
            for item in v:
                out += f"\n[[{name}]]\n" + _toml_text(item, name + ".")
    return out



def case_and_source(case):
    """``(Case, source)``: the case, and the file it came from (for messages) or ''."""
    c = load_case(case)
    source = str(case) if isinstance(case, (str, Path)) and names_a_file(str(case)) else ""
    return c, source



def pick_run(case, run):
    """The run ``run`` (index or name) of a case (TypeError/ValueError naming the runs)."""
    names = [x.name for x in case.run]
    if isinstance(run, bool) or not isinstance(run, (int, str)):
        raise TypeError(f"run = {quote_value(run)}: allowed: a run's index (0 ... {len(names) - 1}) or name ({names})")
    if isinstance(run, int):
        if not 0 <= run < len(names):
            raise ValueError(f"run = {run}: no such run; allowed: 0 ... {len(names) - 1} or a name of {names}")
        return case.run[run]
    r = next((x for x in case.run if x.name == run), None)
    if r is None:
        raise ValueError(f"run = {quote_value(run)}: no run of that name; allowed: {names} or 0 ... {len(names) - 1}")
    return r

