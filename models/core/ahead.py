"""Compiling kernels a run will need later in a second process, while this one compiles others.

numba compiles one function at a time in a process.  A first continuation in the forcing
frequency compiles the event integrator (for its start), then
:func:`~vibeam.models.core.shooting.shoot` with the tangent (its shots), then
:func:`~vibeam.models.core.shooting.correct_frequency` (its corrector, which links and emits the
integrator and the tangent again).  :func:`start` forks a child that compiles kernels of a plan
into numba's on-disk cache while the parent goes on: for the continuation
(:meth:`~vibeam.models.core.shooting.ModalShooting.compile_corrector_ahead`) the tangent and the
corrector's callees that do not call the integrator at once, then, past a :data:`GATE` the
parent opens once it has compiled and cached the integrator (:func:`proceed`), the corrector.  The
parent's shots then load the tangent instead of compiling it, and :func:`wait` (before the
corrector's first call) waits for the child and loads the corrector.  On a 2-core machine the
compilations overlap: a cold ``vibeam continue cases/paper-fig13-continuation.toml --quick``
63.9 -> 37.6 s (``vibeam bench --compile``'s probe, 2026-11-26).

What it does not change: the machine code (the child compiles the same signature with the same
numba configuration and the parent loads what it saved, as any later run would); the results.
If the child fails, is killed, or its cache entry cannot be loaded, the parent compiles the
kernel itself, as without this module.  The child never outlives the parent: it is killed when
the parent exits (an ``atexit`` hook, and on Linux ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` for a
parent that is killed outright), so an interrupted command leaves no compiler behind.

It does nothing (the parent compiles everything, as before) unless all of these hold:

* the platform forks (``os.fork``, Linux: a forked child shares the parent's imported modules
  and compiles at once; elsewhere ``spawn`` would re-import everything);
* this process runs one Python thread (forking a multi-threaded process can deadlock the child:
  a notebook kernel or a dask worker runs several, and compiles everything itself) and may run on
  two cores or more (on one, the child would only take the parent's time);
* the kernel is neither compiled in this process nor in numba's cache (a warm run forks nothing);
* ``VIBEAM_COMPILE_AHEAD`` is not ``0``.

The child drops numba's event listeners it inherited (a progress line or a compile probe of the
parent's must not count its work as the parent's or as a pool worker's); the parent reports the
wait as compiling the kernel (one ``"numba:compile"`` event around the wait and the load), so the
time a user waits is still announced and measured as compiling.  It reads numba's cache through
``Dispatcher._cache`` (numba internals of the pinned range); where those differ, nothing is forked.
"""
from __future__ import annotations

import atexit
import ctypes
import os
import signal
import sys
import threading

from numba import typeof
from numba.core import event

#: dispatcher -> its child's record: {"pid", "gate" (the write end of its pipe, None once opened)}
_PENDING: dict = {}
class _Gate:
    def __repr__(self):
        return "GATE"


#: in a plan (:func:`start`), the child waits here until the parent calls :func:`proceed`
GATE = _Gate()


def enabled() -> bool:
    """Whether :func:`start` may fork (platform, threads, cores, ``VIBEAM_COMPILE_AHEAD``)."""
    return (os.environ.get("VIBEAM_COMPILE_AHEAD", "1") != "0" and hasattr(os, "fork")
            and sys.platform.startswith("linux") and threading.active_count() == 1 and _cores() >= 2)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _signature(args) -> tuple:
    return tuple(typeof(a) for a in args)


def _load_cached(dispatcher, sig) -> bool:
    """Whether the kernel is compiled here for ``sig`` or loads from numba's cache (then loaded, as
    numba's own ``Dispatcher.compile`` does on a cache hit)."""
    if sig in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    if cache is None:
        return False
    cres = cache.load_overload(sig, dispatcher.targetctx)
    if cres is None:
        return False
    if not cres.objectmode:
        dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
    dispatcher.add_overload(cres)
    return True


_STATE = {"atexit": False}


def _tie_to(parent: int) -> None:
    """In a child: be killed when ``parent`` exits (Linux ``prctl(PR_SET_PDEATHSIG, SIGKILL)``),
    and leave at once if it has exited already."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)     # a Ctrl-C of the terminal ends the child too
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):                # not Linux's libc: the atexit hook alone
        pass
    if os.getppid() != parent:                       # the parent exited before the prctl
        os._exit(1)


def end_children() -> None:
    """Kill and reap every child :func:`start` forked that is still compiling (run at exit)."""
    for record in list(_PENDING.values()):
        if record.get("done") or record.get("owner") != os.getpid():   # not a forked worker's business
            continue
        try:
            os.kill(record["pid"], signal.SIGKILL)
            os.waitpid(record["pid"], 0)
        except (OSError, ChildProcessError):
            pass
        record["done"] = True
    _PENDING.clear()


def _child(plan, gate_r) -> int:
    for listeners in getattr(event, "_registered", {}).values():
        listeners.clear()          # the parent's progress lines and probes are not about this process
    for item in plan:
        if item is GATE:
            if os.read(gate_r, 1) != b"1":       # closed without a go: the parent no longer needs it
                return 0
            continue
        dispatcher, sig = item
        dispatcher.compile(sig)                  # compiled and saved to numba's cache
    return 0


def start(plan, signatures: bool = False) -> bool:
    """Fork a child that compiles kernels into numba's cache, in the order of ``plan``.

    Parameters
    ----------
    plan : sequence
        ``(dispatcher, args)`` pairs (a kernel with ``cache=True`` and arguments of the types it
        will be called with; their values are not used), and at most one :data:`GATE`: the child
        compiles what follows it only after :func:`proceed` (e.g. once the parent has compiled and
        cached a callee they share, so that the child loads it instead of compiling it again).
    signatures : bool, optional
        The pairs hold numba signatures (tuples of numba types) instead of arguments.

    Returns
    -------
    bool
        True when a child was started; False when nothing was done: not :func:`enabled`, a child
        is compiling one of these kernels already, every kernel is compiled or cached, or the
        check failed (numba's internals differ).
    """
    _reap()
    if not enabled() or any(item is not GATE and item[0] in _PENDING for item in plan):
        return False
    try:
        todo = []
        for item in plan:
            if item is GATE:
                todo.append(GATE)
                continue
            dispatcher, args = item
            sig = tuple(args) if signatures else _signature(args)
            if not _load_cached(dispatcher, sig):
                todo.append((dispatcher, sig))
    except Exception:
        return False
    while todo and todo[-1] is GATE:
        todo.pop()
    if not todo:
        return False
    gate_r, gate_w = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:                                   # the child: compile, save, leave
        code = 1
        try:
            _tie_to(parent)
            os.close(gate_w)
            code = _child(todo, gate_r)
        except BaseException:
            pass
        finally:
            os._exit(code)
    os.close(gate_r)
    if not _STATE["atexit"]:
        atexit.register(end_children)
        _STATE["atexit"] = True
    record = {"pid": pid, "gate": gate_w if GATE in todo else None, "owner": parent}
    if record["gate"] is None:
        os.close(gate_w)
    for item in todo:
        if item is not GATE:
            _PENDING[item[0]] = record
    return True


def _reap() -> None:
    """Forget the kernels of children that have ended (their kernels are in the cache or not)."""
    for d, record in list(_PENDING.items()):
        if record.get("done"):
            _PENDING.pop(d, None)
            continue
        try:
            pid, _status = os.waitpid(record["pid"], os.WNOHANG)
        except ChildProcessError:
            pid = record["pid"]
        if pid == record["pid"]:
            record["done"] = True
            if record["gate"] is not None:
                os.close(record["gate"])
                record["gate"] = None
            _PENDING.pop(d, None)


def proceed(dispatcher) -> None:
    """Let the child compiling ``dispatcher`` go past its :data:`GATE` (nothing if none)."""
    record = _PENDING.get(dispatcher)
    if record is not None:
        _open(record)


def wait(dispatcher, args) -> None:
    """Before ``dispatcher``'s first call with ``args``: wait for the child :func:`start` forked for
    it (if any), reported to numba's event listeners as compiling it, then load what it saved (or
    compile it here if it saved nothing)."""
    record = _PENDING.pop(dispatcher, None)
    if record is None:
        return
    _open(record)
    sig = _signature(args)
    with event.trigger_event("numba:compile", data=dict(dispatcher=dispatcher, args=sig, return_type=None)):
        try:
            os.waitpid(record["pid"], 0)
        except ChildProcessError:        # reaped already (another kernel of the same child)
            pass
        dispatcher.compile(sig)          # a cache hit; compiled here only if the child saved nothing


def _open(record) -> None:
    if record["gate"] is not None:
        try:
            os.write(record["gate"], b"1")
        except OSError:
            pass
        os.close(record["gate"])
        record["gate"] = None


def pending() -> dict:
    """``{dispatcher: pid}``: the kernels a child is compiling, and its process id."""
    return {d: r["pid"] for d, r in _PENDING.items()}
