"""vibeam's exceptions and the wording of their messages.

Every framework module may import this one: it imports nothing of vibeam.  The classes are
re-exported where they were defined first (``vibeam.case.schema.CaseError``,
``vibeam.case.schema.InputError``, ``vibeam.cli.Terminated``).
:class:`vibeam.models.orbits.continuation.ContinuationError` stays with the models, which never import
the framework.

The signal a command records (:class:`RecordingHandler`, :func:`recording_signals`) is here too:
every layer of the framework asks :func:`signal_recorded` before it replaces a complete file.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading


class CaseError(ValueError):
    """A case file that cannot be used; the message names key, value and what is allowed."""


class InputError(CaseError):
    """Other input that cannot be used (a file or folder, a command-line value); the message
    names the file, option or key and what is allowed.  The command line reports it like a
    :class:`CaseError`: one line ``vibeam: error: ...`` and exit code 2."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the same clean-up runs (exit code 143)."""


# ----------------------------------------------------------------------------- signals
class RecordingHandler:
    """The handler of SIGINT or SIGTERM while a command runs: it records the signal, then
    raises its interrupt (through ``then(signum, frame)`` when given, e.g. Python's
    :func:`signal.default_int_handler`) -- except inside an import or numba's / llvmlite's own
    Python code (:func:`inside_internals`), where it only records: the interrupt is raised at
    the next check (the models' loops and numba's compiler passes, a file's commit, the
    command's end).

    The record outlives the exception: where compiled code or a broad ``except`` swallows
    the interrupt, :func:`vibeam.models.interrupts.check` (the models' loops) and
    :func:`signal_recorded` (the commit of a results file, the command's exit code) still
    see it (issue 57).

    Attributes
    ----------
    recorded : type or None
        ``exc`` once the signal has arrived (the protocol :mod:`vibeam.models.interrupts`
        reads through :func:`signal.getsignal`), None before.
    """

    def __init__(self, exc: type, then=None):
        self.exc = exc
        self.then = then
        self.recorded: type | None = None

    def __call__(self, signum, frame):
        self.recorded = self.exc            # first: whatever happens to the exception below
        if inside_internals(frame):
            # not raised inside a module being imported or numba's / llvmlite's own Python code
            # (a cache load, a boxing's _numba_unpickle): recorded only, it is raised at the next
            # check of the models' loops and numba's compiler passes (vibeam.models.interrupts), of
            # a file's commit (stop_if_signalled) and at the command's end
            return
        if self.then is not None:
            self.then(signum, frame)
        raise self.exc()


def _generated_new(code) -> bool:
    """Whether ``code`` is a generated ``__new__``: a NamedTuple's (``collections.namedtuple``
    evaluates ``lambda _cls, ...`` in ``<string>``) or another one made by ``exec``."""
    return code.co_filename.startswith("<") and (
        code.co_name == "__new__" or (code.co_name == "<lambda>" and code.co_varnames[:1] == ("_cls",)))


def _library_dirs() -> tuple:
    dirs = []
    for name in ("numba", "llvmlite"):
        mod = sys.modules.get(name)
        for d in getattr(mod, "__path__", None) or ():
            dirs.append(os.path.join(d, ""))
    return tuple(dirs)


def inside_internals(frame) -> bool:
    """Whether ``frame`` (where a signal's handler runs) or one of its callers is a module being
    imported or numba's or llvmlite's own Python code, or ``frame`` is a generated ``__new__`` (a
    NamedTuple's, which numba's boxing of a record result calls), where an exception raised by a
    signal could leave native state half made (a module's numba extensions half registered, a cache
    entry half loaded, a boxed result half built).

    A boxed result half built is a crash, not an error: the exception raised in a Python function
    that compiled code calls while it boxes its results (numba's ``_numba_unpickle`` for each
    array's type) can be cleared by the next such call, and the result tuple then reaches Python
    with a NULL item and no exception set: unpacking it dereferences NULL (SIGSEGV: once in 300
    SIGTERMs sent to ``vibeam continue`` under a test's wrapper of ``_numba_unpickle`` that lay
    outside numba's directory; the core held the compiled corrector's result with its fifth item
    NULL).

    Parameters
    ----------
    frame : frame or None
        The frame the handler received.

    Returns
    -------
    bool
        True where the handler should only record the signal.
    """
    dirs = _library_dirs()
    if frame is not None and _generated_new(frame.f_code):
        return True
    while frame is not None:
        name = frame.f_code.co_filename
        if name.startswith("<frozen importlib") or (dirs and name.startswith(dirs)):
            return True
        frame = frame.f_back
    return False


#: the signals a command records, and the interrupt of each
_SIGNALS = tuple((getattr(signal, name), exc) for name, exc in (("SIGINT", KeyboardInterrupt), ("SIGTERM", Terminated))
                 if hasattr(signal, name))


@contextlib.contextmanager
def recording_signals(then=None):
    """Install a :class:`RecordingHandler` for SIGINT and SIGTERM for the block, then restore
    the handlers it found.

    SIGINT keeps what it was when ignored (``SIG_IGN``: a background job) or left to the
    system (``SIG_DFL``), and calls the handler it found after recording (Python's own
    raises ``KeyboardInterrupt``).  SIGTERM raises :class:`Terminated` (exit code 143),
    after ``then[SIGTERM](signum, frame)`` when given.  Off the main thread (a program that
    embeds vibeam) nothing is installed.

    Parameters
    ----------
    then : dict, optional
        ``{signal number: callable(signum, frame)}`` run after recording, before the raise.

    Yields
    ------
    list of RecordingHandler
        The handlers installed (what they recorded stays readable after the block).
    """
    installed: list = []
    if threading.current_thread() is not threading.main_thread():
        yield installed
        return
    then = dict(then or {})
    old = {}
    try:
        for s, exc in _SIGNALS:
            prev = signal.getsignal(s)
            if s == signal.SIGINT:
                if not callable(prev):
                    continue
                then.setdefault(s, prev)
            old[s] = prev
            installed.append(RecordingHandler(exc, then.get(s)))
            signal.signal(s, installed[-1])
        yield installed
    finally:
        for s, prev in old.items():
            signal.signal(s, prev if prev is not None else signal.SIG_DFL)


def signal_recorded() -> type | None:
    """The interrupt (``KeyboardInterrupt`` or :class:`Terminated`) of a signal that the
    installed :class:`RecordingHandler` recorded, or None."""
    for s, _ in _SIGNALS:
        exc = getattr(signal.getsignal(s), "recorded", None)
        if exc is not None:
            return exc
    return None


def stop_if_signalled() -> None:
    """Raise the interrupt of a recorded signal, or of one that arrived while SIGINT/SIGTERM
    are blocked (:func:`signal.sigpending`; its handler runs now): the last look before a
    complete file replaces the old one, so that a signal never ends in a replaced file.

    Raises
    ------
    KeyboardInterrupt
        Or :class:`Terminated`.
    """
    if hasattr(signal, "sigpending") and threading.current_thread() is threading.main_thread():
        held = signal.sigpending() & {s for s, _ in _SIGNALS}
        if held:
            # unblocked, its handler runs at once (CPython checks the signals on return)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, held)
    exc = signal_recorded()
    if exc is not None:
        raise exc()


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
