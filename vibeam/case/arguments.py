"""Arguments of the command line and of the Python API, checked by the rules of the case files.

The Python API (:mod:`vibeam.api`) validates its arguments like the command line validates
its options and a case file its keys: a value of the wrong type raises :class:`TypeError`,
a value out of range :class:`ValueError`, each with one line naming the argument, the value
and what is allowed.  A number that is also a case key (``periods`` is ``[sweep]
record_periods``, ``transient`` is ``transient_periods``, ``Omega`` a point of ``[sweep]
Omega``) is checked by that key's own validator (:func:`check_case_value`, :func:`check_frequency`),
so the two cannot drift apart.

Workers: ``--jobs`` / ``jobs`` is a whole number from 1 to :func:`max_jobs`, at most
:data:`JOBS_PER_CORE` workers per core of the machine (``os.cpu_count()``): a sweep line is
CPU-bound, so more workers than cores only share the cores, and thousands of processes would
exhaust the machine's memory and process table before any point is computed.
"""
from __future__ import annotations

import argparse
import numbers
import os

from vibeam.errors import quote_value

#: workers allowed per core (``--jobs``, ``jobs``): see the module docstring
JOBS_PER_CORE = 4


def max_jobs() -> int:
    """The most workers a run may ask for: :data:`JOBS_PER_CORE` x ``os.cpu_count()``."""
    return JOBS_PER_CORE * (os.cpu_count() or 1)


def _jobs_allowed() -> str:
    cores = os.cpu_count() or 1
    return (f"a whole number from 1 to {max_jobs()} ({JOBS_PER_CORE} x the {cores} core{'s' if cores != 1 else ''} "
            f"of this machine)")


def _scalar(value):
    """A numpy scalar as the Python number it holds; anything else as it is."""
    if type(value).__module__ == "numpy" and hasattr(value, "item") and getattr(value, "ndim", None) == 0:
        return value.item()
    return value


def check_jobs(jobs, name: str = "jobs", none: str = "None: all cores"):
    """``jobs`` as an int from 1 to :func:`max_jobs`, or None.

    Raises
    ------
    TypeError
        Not a whole number (a float, a string, a bool).
    ValueError
        Below 1 or above :func:`max_jobs`.
    """
    jobs = _scalar(jobs)
    if jobs is None:
        return None
    allowed = _jobs_allowed() + (f", or {none}" if none else "")
    if isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral):
        raise TypeError(f"{name} = {quote_value(jobs)}: not a whole number; allowed: {allowed}")
    if not 1 <= int(jobs) <= max_jobs():
        raise ValueError(f"{name} = {int(jobs)} is not allowed; allowed: {allowed}")
    return int(jobs)


def check_whole(value, name: str, lo: int, hi: int) -> int:
    """``value`` as an int in ``[lo, hi]`` (TypeError for anything but a whole number,
    ValueError outside the range; one line naming the argument, the value and what is allowed)."""
    value = _scalar(value)
    allowed = f"a whole number from {lo} to {hi}"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} = {quote_value(value)}: not a whole number; allowed: {allowed}")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name} = {int(value)} is not allowed; allowed: {allowed}")
    return int(value)


def jobs_option(text: str) -> int:
    """argparse type of ``--jobs``: :func:`check_jobs` of a whole number."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number; allowed: {_jobs_allowed()}") from None
    try:
        return check_jobs(v, "--jobs", none="")
    except ValueError:
        raise argparse.ArgumentTypeError(f"{v} is not allowed; allowed: {_jobs_allowed()}") from None


def check_path(value, name: str, optional: bool = True):
    """A path argument (str or os.PathLike) that is not empty; None when ``optional``.

    Raises
    ------
    TypeError
        Not a str or path.
    ValueError
        An empty or blank string (which would silently mean the current folder).
    """
    if value is None and optional:
        return None
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} = {quote_value(value)}: not a path; allowed: a str or pathlib.Path"
                        + (", or None" if optional else ""))
    if not str(os.fspath(value)).strip():
        raise ValueError(f"{name} = {quote_value(value)}: an empty path; allowed: a folder or file name"
                         + (" (or None for the default)" if optional else ""))
    return value


def path_option(option: str):
    """argparse type of a path option (``--out``, ``--write``, ...): not empty."""
    def conv(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{text!r} is an empty path; allowed: a folder or file name "
                                             f"(leave {option} out for the default)")
        return text
    conv.__name__ = "path"
    return conv


def check_flag(value, name: str) -> bool:
    """A bool argument (``True`` / ``False``); 0 and 1 are not taken for it.

    Raises
    ------
    TypeError
        Anything else.
    """
    value = _scalar(value)
    if not isinstance(value, bool):
        raise TypeError(f"{name} = {quote_value(value)}: allowed: True or False")
    return value


def _describe(annotation, metadata=()) -> str:
    """What a case key's annotation allows, in words (``a whole number >= 1``)."""
    import typing  # lazy: keeps typing out of `vibeam --help`

    from annotated_types import Ge, Gt, Le, Lt  # lazy: keeps annotated_types and typing out of `vibeam --help`

    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        base, *meta = typing.get_args(annotation)
        return _describe(base, [*meta, *metadata])
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", typing.Union)):
        return " or ".join(_describe(a) for a in typing.get_args(annotation) if a is not type(None))
    if origin is typing.Literal:
        return " or ".join(repr(a) for a in typing.get_args(annotation))
    words = {int: "a whole number", float: "a finite number", bool: "True or False", str: "a string"}
    out = words.get(annotation, getattr(annotation, "__name__", str(annotation)))
    bounds = []
    for m in metadata:
        for c in [m, *getattr(m, "metadata", ())]:      # a FieldInfo inside Annotated holds its own
            for cls, op, attr in ((Ge, ">=", "ge"), (Gt, ">", "gt"), (Le, "<=", "le"), (Lt, "<", "lt")):
                if isinstance(c, cls):
                    bounds.append(f"{op} {getattr(c, attr)}")
    return out + (" " + " and ".join(bounds) if bounds else "")


_ADAPTERS: dict = {}


def check_case_value(value, name: str, table, key: str):
    """``value`` checked by the validator of the case key ``key`` of ``table`` (a spec class of
    :mod:`vibeam.case.schema`, e.g. :class:`~vibeam.case.schema.SweepSpec`): the same types, ranges and
    strictness (no NaN, no infinity, no bool for a number) as in a case file.

    Returns
    -------
    The validated value.

    Raises
    ------
    TypeError
        A value of a type the key does not take.
    ValueError
        A value out of the key's range; the message names the argument, the value, what is
        allowed and the case key whose rule it is.
    """
    from typing import Annotated  # lazy: keeps typing out of `vibeam --help`

    # lazy: keeps pydantic (43 modules) out of `vibeam --help`
    from pydantic import ConfigDict, TypeAdapter, ValidationError

    value = _scalar(value)
    f = table.model_fields[key]
    if (table, key) not in _ADAPTERS:
        ann = Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
        _ADAPTERS[table, key] = TypeAdapter(ann, config=ConfigDict(strict=True, allow_inf_nan=False))
    try:
        return _ADAPTERS[table, key].validate_python(value)
    except ValidationError as e:
        types = [x["type"] for x in e.errors()]
        wrong_type = all(t.endswith("_type") or (t == "literal_error" and not isinstance(value, str)) for t in types)
        allowed = _describe(f.annotation, f.metadata)
        where = getattr(table, "__doc__", "") or ""
        section = where.split("``")[1] if where.count("``") >= 2 else table.__name__
        msg = f"{name} = {quote_value(value)}: allowed: {allowed} (the rule of {section} {key} in a case file)"
        raise (TypeError if wrong_type else ValueError)(msg) from None


def case_value_option(option: str, table: str, key: str):
    """argparse type of an option that overrides a case key (``--atol`` is ``[regress]
    amplitude_atol``): a float checked by that key's own rule (:func:`check_case_value`), so
    ``nan``, ``inf`` and values out of range are refused in one line (exit 2) like in a case file.
    ``table`` is the name of a spec class of :mod:`vibeam.case.schema` (``"RegressSpec"``)."""
    def conv(text: str) -> float:
        from vibeam.case import schema  # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`

        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        try:
            return check_case_value(v, option, getattr(schema, table), key)
        except (TypeError, ValueError) as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    conv.__name__ = "number"
    return conv


def check_frequency(value, name: str = "Omega", key: str = "Omega"):
    """A forcing frequency (``Omega``, or ``frequency_hz`` in Hz): a finite number > 0, the rule
    of a point of ``[sweep] Omega`` / ``frequency_hz`` (:func:`vibeam.case.schema.check_grid`).

    Raises
    ------
    TypeError
        Not a real number (a bool, a string, a complex number).
    ValueError
        NaN, infinite, zero or negative.
    """
    # lazy: keeps the case schema (pydantic, numba: 0.4 s) out of `vibeam --help`
    from vibeam.case.schema import OMEGA_MAX, check_grid

    value = _scalar(value)
    allowed = f"a finite number > 0 (a point of [sweep] {key})"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} = {quote_value(value)}: not a number; allowed: {allowed}")
    try:
        check_grid([float(value), float(value), 1], positive=True)
    except ValueError:
        raise ValueError(f"{name} = {quote_value(value)} is not allowed; allowed: {allowed}") from None
    if key == "Omega" and float(value) > OMEGA_MAX:
        raise ValueError(f"{name} = {quote_value(value)} is above Omega's limit; allowed: a number > 0 and <= "
                         f"{OMEGA_MAX:g} (the exact flows' Omega^4 terms overflow double precision)")
    return float(value)
