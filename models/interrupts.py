"""Ctrl-C (or SIGTERM) that arrives while a compiled kernel runs.

Python runs its signal handler when control returns to the interpreter; if that is inside a
numba-compiled call, the ``KeyboardInterrupt`` it raises can come back wrapped: ``SystemError:
<built-in method ...> returned a result with an exception set``, the interrupt as its
``__cause__`` or ``__context__``.  Code that turns a failing call into a ``failed`` status
(a shot, a point, a start) must hand such an exception on as the interrupt it is: otherwise a
user's Ctrl-C ends as a ``failed`` point in a file marked complete.
"""
from __future__ import annotations


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


def reraise_interrupt(exc: BaseException) -> None:
    """Raise the interrupt in ``exc``'s chain (:func:`interrupt_of`), if there is one."""
    ki = interrupt_of(exc)
    if ki is not None:
        raise ki
