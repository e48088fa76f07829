"""How long numba spends compiling kernels for first use, measured apart from run times.

numba compiles a kernel the first time it is called with new argument types and keeps the
machine code in its cache (``__pycache__``, or ``NUMBA_CACHE_DIR``), so a first run on a fresh
install pays seconds that no later run pays.  :class:`CompileClock` listens to numba's
``"numba:compile"`` events (numba's event API, ``numba.core.event``) in this process and sums the
outermost compilations, so that the sweep engine can report that time once, in one line, and
subtract it from the run times it prints and stores.  Compilations in other processes (pool
workers) are not seen here: the engine loads the kernels before it starts a pool, so that
workers inherit them.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from numba.core import event

from vibeam.errors import InputError
from vibeam.io.outdir import replace_file

#: compile seconds of the entry points a first run meets, measured by ``vibeam bench --compile`` on
#: the development machine (2 cores, 2026-11-26, with a second process compiling beside the first
#: (:mod:`vibeam.models.core.ahead`): the integrator's callees, the continuation's tangent and
#: corrector; ``shoot`` then loads the tangent and ``correct_frequency`` is the wait for the rest):
#: the expected time said before a compile when this machine has measured none
#: (:func:`expected_seconds`)
MEASURED_S = {
    "integrate_work [Newton stops only]": 15.7,
    "integrate_work [with compliant stops (linear contact phases)]": 30.7,
    "substeps": 0.1,
    "new_work": 0.6,
    "shoot": 9.0,
    "correct_frequency": 3.7,
    "tangent": 20.0,
}


def specialisation(kernel: str, args) -> str:
    """A readable name of a compiled specialisation: the event integrator's (``integrate_work``) by
    its compliant data (``cw``: None for a scene of Newton stops only; else the kinds of contact
    phase compiled, :class:`vibeam.models.core.phases.Compliant`'s ``lin`` and ``itab``: a second
    ``ContactPhases`` or ``Tableau`` beside ``ph`` and ``tab``), any other by its signature.

    Parameters
    ----------
    kernel : str
        The kernel's qualified name (``vibeam.models.core.integrator.integrate_work``).
    args : sequence of str
        Its argument types as numba prints them.
    """
    args = [str(a) for a in args]
    if kernel.endswith("integrate_work") and len(args) > 3:
        if args[3] == "none":
            return "Newton stops only"
        kinds = [k for k, t in (("linear", "ContactPhases("), ("Runge-Kutta", "Tableau(")) if args[3].count(t) > 1]
        return f"with compliant stops ({' and '.join(kinds) or 'no'} contact phases)"
    sig = "(" + ", ".join(args) + ")"
    return sig if len(sig) <= 120 else sig[:120] + " ...)"


def entry_name(kernel: str, args) -> str:
    """``"<function> [<specialisation>]"`` for the event integrator, else the function's name."""
    short = kernel.rsplit(".", 1)[-1]
    return f"{short} [{specialisation(kernel, args)}]" if short == "integrate_work" else short


def times_file() -> Path:
    """Where this machine's compile times are kept: beside numba's cache (``NUMBA_CACHE_DIR``), else
    in ``$XDG_CACHE_HOME/vibeam`` (``~/.cache/vibeam``)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "vibeam")
    return Path(base) / "vibeam-compile-times.json"


def _read_times() -> dict:
    try:
        d = json.loads(times_file().read_text())
        return {str(k): float(v) for k, v in d.items()} if isinstance(d, dict) else {}
    except (OSError, ValueError, TypeError):
        return {}


def expected_seconds(name: str) -> tuple[float | None, str]:
    """``(seconds, source)`` expected to compile entry point ``name``: the last measurement on this
    machine (``"measured here"``), else :data:`MEASURED_S` (``"measured on a 2-core machine"``), else
    ``(None, "")``."""
    t = _read_times().get(name)
    if t is not None:
        return t, "last time on this machine"
    t = MEASURED_S.get(name)
    return (t, "on a 2-core machine") if t is not None else (None, "")


def record_seconds(name: str, seconds: float) -> None:
    """Keep ``seconds`` as this machine's compile time of ``name`` (written whole by
    :func:`vibeam.io.outdir.replace_file`; a file that cannot be written is skipped, the figure is
    only a hint)."""
    path = times_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        d = _read_times()
        d[name] = round(float(seconds), 2)
        replace_file(path, json.dumps(d, indent=1, sort_keys=True))
    except (OSError, InputError):
        pass


class CompileClock:
    """Context manager: ``seconds`` spent compiling (outermost compilations) and ``count`` of
    specialisations compiled while it was open.

    ``notice`` (a callable, optional) is called as ``notice(name, expected_s, source)`` when an
    outermost compilation starts -- loading a kernel from numba's cache is not one -- so that a first
    run says what it compiles, and about how long it takes, before the wait, not after it (issue 44);
    ``done`` as ``done(name, seconds)`` when it ends.  Each entry point's time is kept
    (:func:`record_seconds`) as the next expectation on this machine.

    Examples
    --------
    >>> with CompileClock() as c:            # doctest: +SKIP
    ...     run_something()
    >>> c.seconds, c.count
    """

    def __init__(self, notice=None, done=None):
        self.seconds = 0.0
        self.count = 0
        self.entries = []          # (name, seconds) of the outermost compilations, in order
        self._depth = 0
        self._t0 = 0.0
        self._name = ""
        self._listener = None
        self._notice = notice
        self._done = done

    def __enter__(self):
        clock = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                if clock._depth == 0:
                    clock._t0 = time.perf_counter()
                    data = ev.data or {}
                    py = getattr(data.get("dispatcher"), "py_func", None)
                    kernel = f"{getattr(py, '__module__', '?')}.{getattr(py, '__qualname__', '?')}"
                    clock._name = entry_name(kernel, data.get("args") or ())
                    if clock._notice is not None:      # said when the compilation starts
                        clock._notice(clock._name, *expected_seconds(clock._name))
                clock._depth += 1

            def on_end(self, ev):
                clock._depth -= 1
                clock.count += 1
                if clock._depth == 0:
                    dt = time.perf_counter() - clock._t0
                    clock.seconds += dt
                    clock.entries.append((clock._name, dt))
                    record_seconds(clock._name, dt)
                    if clock._done is not None:
                        clock._done(clock._name, dt)

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc):
        event.unregister("numba:compile", self._listener)
        return False
