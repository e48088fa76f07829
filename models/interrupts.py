"""Ctrl-C (or SIGTERM) that arrives while a compiled kernel runs.

Python runs its signal handler when control returns to the interpreter; if that is inside a
numba-compiled call, the ``KeyboardInterrupt`` it raises can come back wrapped: ``SystemError:
<built-in method ...> returned a result with an exception set``, the interrupt as its
``__cause__`` or ``__context__``.  Code that turns a failing call into a ``failed`` status
(a shot, a point, a start) must hand such an exception on as the interrupt it is: otherwise a
user's Ctrl-C ends as a ``failed`` point in a file marked complete.

It can also be lost altogether: the handler runs inside a Python function that compiled code
calls (numba's ``_numba_unpickle``, from the compiled continuation corrector), and the
compiled caller drops the exception (issue 57: a continuation ran 30 s past Ctrl-C and
replaced its results file).  So the handler a command installs *records* the signal before
it raises (:mod:`vibeam.interrupts`): the handler object carries the exception class to raise
in its attribute ``recorded`` (None until its signal arrives), read here through
:func:`signal.getsignal` -- the models never import the framework.  :func:`check` raises a
recorded signal again; it is called at every loop boundary of the models (a shot, a
corrector call, a continuation step) and by :func:`reraise_interrupt`, which every broad
``except`` that turns an error into a status calls, so a swallowed interrupt stops the work
at its next step.  Without such a handler (the API in a program of its own) both do what
Python's own handler does.

numba's compiler swallows it too: a handler that runs inside llvmlite's object-cache callback
(a ``ctypes`` callback: "Exception ignored on calling ctypes callback function") is lost, and the
compile went on for 89 s.  So :func:`check` also runs before and after every compiler pass
(numba's ``"numba:run_pass"`` events, registered on import), where a recorded signal stops the
compile.
"""
from __future__ import annotations

import signal

from numba.core import event

#: the signals whose handlers may record (SIGTERM does not exist everywhere)
SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM") if hasattr(signal, name))


def pending() -> type | None:
    """The exception class of a signal that the installed handler recorded (``recorded``
    attribute of the handler of SIGINT, then of SIGTERM), or None.

    A handler without that attribute (Python's own, ``SIG_IGN``, ``SIG_DFL``) records nothing."""
    for s in SIGNALS:
        exc = getattr(signal.getsignal(s), "recorded", None)
        if exc is not None:
            return exc
    return None


def check() -> None:
    """Raise the interrupt of a recorded signal (:func:`pending`), if there is one.

    Raises
    ------
    KeyboardInterrupt
        Or its subclass that the handler records (SIGTERM: ``vibeam.errors.Terminated``)."""
    exc = pending()
    if exc is not None:
        raise exc()


def interrupt_of(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The ``KeyboardInterrupt`` (or a subclass, e.g. SIGTERM's) in ``exc``'s chain of causes
    and contexts, or None."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ if exc.__cause__ is not None else exc.__context__
    return None


def reraise_interrupt(exc: BaseException | None = None) -> None:
    """Raise the interrupt in ``exc``'s chain (:func:`interrupt_of`), if there is one, else a
    recorded one (:func:`check`): call it first in every ``except`` that turns an error
    into a status."""
    ki = interrupt_of(exc)
    if ki is not None:
        raise ki
    check()


class _CompileCheck(event.Listener):
    """A recorded signal stops numba's compiler between two passes (module docstring)."""

    def on_start(self, ev):
        check()

    def on_end(self, ev):
        check()


event.register("numba:run_pass", _CompileCheck())
