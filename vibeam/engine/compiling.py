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
import stat
import time
from pathlib import Path

from numba.core import event

from vibeam.errors import InputError
from vibeam.io.outdir import replace_file

#: compile seconds of the entry points a first run meets, measured by ``vibeam bench --compile`` on
#: the development machine (2 cores, 1-minute load average about 1, 2026-11-26, numba 0.68.1, with
#: the continuation's tangent and corrector compiled beside it (:mod:`vibeam.models.core.ahead`);
#: ``shoot`` then loads the tangent and ``correct_frequency`` is the wait for the rest): the expected
#: time said before a compile when this machine has measured none (:func:`expected_seconds`)
MEASURED_S = {
    "integrate_work [Newton stops only]": 19.8,
    "integrate_work [with compliant stops (linear contact phases)]": 37.9,
    "substeps": 0.1,
    "new_work": 0.6,
    "shoot": 9.0,
    "correct_frequency": 3.7,
    "tangent": 20.0,
}
#: the host of :data:`MEASURED_S`
MEASURED_ON = "the development machine: 2 cores at load 1"


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
    in the user cache folder ``$XDG_CACHE_HOME/vibeam`` (``~/.cache/vibeam``; README, "Cold
    compile")."""
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "vibeam")
    return Path(base) / "vibeam-compile-times.json"


def load() -> tuple[float | None, int]:
    """``(1-minute load average or None where the platform has none, cores this process may use)``."""
    try:
        la = os.getloadavg()[0]
    except (AttributeError, OSError):
        la = None
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return la, cores


def _read_times() -> dict:
    """``{name: {"seconds", "load", "cores"}}`` of this machine's file; {} if it is missing, not a
    regular file (a FIFO would block the open: issue 57), too large or unreadable."""
    path = times_file()
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError:
        return {}
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > 1 << 20:
            return {}
        with os.fdopen(fd, "rb", closefd=False) as f:
            d = json.loads(f.read().decode())
    except (OSError, ValueError, TypeError, UnicodeDecodeError):
        return {}
    finally:
        os.close(fd)
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            try:
                v = v if isinstance(v, dict) else {"seconds": v}
                la = v.get("load")
                out[str(k)] = {"seconds": float(v["seconds"]), "load": None if la is None else float(la),
                               "cores": int(v.get("cores") or 0)}
            except (KeyError, TypeError, ValueError, AttributeError):
                continue
    return out


def _host(la, cores) -> str:
    return f"{cores} cores at load {la:.1f}" if la is not None and cores else "load unknown"


def expected_seconds(name: str) -> tuple[float | None, str]:
    """``(seconds, source)`` expected to compile entry point ``name``: the last measurement on this
    machine, with the load it had then (``"last time here, 2 cores at load 0.4"``), else
    :data:`MEASURED_S` (``"on the development machine: 2 cores at load 1"``), else ``(None, "")``.
    The load average now is added where it is more than twice the cores' (the wait grows with it)."""
    la_now, cores_now = load()
    now = f"; load now {la_now:.1f}" if la_now is not None and la_now > 2 * cores_now else ""
    t = _read_times().get(name)
    if t is not None:
        return t["seconds"], f"last time here, {_host(t['load'], t['cores'])}{now}"
    s = MEASURED_S.get(name)
    return (s, f"on {MEASURED_ON}{now}") if s is not None else (None, "")


def record_seconds(name: str, seconds: float, at_load: tuple | None = None) -> None:
    """Keep ``seconds`` as this machine's compile time of ``name``, with the load average and cores
    ``at_load`` (:func:`load` at the compile's start; now if None), written whole by
    :func:`vibeam.io.outdir.replace_file`; a file that cannot be written is skipped (the figure is
    only a hint)."""
    path = times_file()
    la, cores = at_load if at_load is not None else load()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        d = _read_times()
        d[name] = {"seconds": round(float(seconds), 2), "load": None if la is None else round(la, 2),
                   "cores": int(cores)}
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
        self._load = (None, 1)
        self._listener = None
        self._notice = notice
        self._done = done

    def __enter__(self):
        clock = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                if clock._depth == 0:
                    clock._t0 = time.perf_counter()
                    clock._load = load()
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
                    record_seconds(clock._name, dt, clock._load)
                    if clock._done is not None:
                        clock._done(clock._name, dt)

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc):
        event.unregister("numba:compile", self._listener)
        return False
