"""vibeam's exceptions and the wording of their messages.

Every framework module may import this one: it imports nothing of vibeam.  The classes are
re-exported where they were defined first (``vibeam.case.schema.CaseError``,
``vibeam.case.schema.InputError``, ``vibeam.io.results.ForeignFileError``, ``vibeam.cli.Terminated``).
:class:`vibeam.models.continuation.ContinuationError` stays with the models, which never import
the framework.
"""
from __future__ import annotations


class CaseError(ValueError):
    """A case file that cannot be used; the message names key, value and what is allowed."""


class InputError(CaseError):
    """Other input that cannot be used (a file or folder, a command-line value); the message
    names the file, option or key and what is allowed.  The command line reports it like a
    :class:`CaseError`: one line ``vibeam: error: ...`` and exit code 2."""


class ForeignFileError(ValueError):
    """A results file that belongs to another case (written by another process meanwhile)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the same clean-up runs (exit code 143)."""


# ----------------------------------------------------------------------------- message wording
#: the longest value (its repr) that a message quotes in full
MAX_VALUE_CHARS = 80


def one_line(text: str) -> str:
    """``text`` on one line: line breaks and other unprintable characters escaped."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def quote_value(v) -> str:
    """A value as quoted in messages: its repr, on one line, shortened."""
    try:
        r = repr(v)
    except Exception:  # pragma: no cover - TOML values always have a repr
        r = f"<{type(v).__name__}>"
    if len(r) > MAX_VALUE_CHARS:
        r = r[: MAX_VALUE_CHARS - 3] + "..."
    return one_line(r)


def case_error(msg: str) -> CaseError:
    """A :class:`CaseError` whose message is ``msg`` on one line (see :func:`one_line`)."""
    return CaseError(one_line(msg))
