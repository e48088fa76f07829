"""Compiling kernels a run will need later in a second process, while this one compiles others.

numba compiles one function at a time in a process.  A first continuation in the forcing
frequency compiles the event integrator (for its start), then
:func:`~vibeam.models.core.shooting.shoot` with the tangent (its shots), then
:func:`~vibeam.models.core.shooting.correct_frequency` (its corrector, which links and emits the
integrator and the tangent again).  :func:`start` forks a child that compiles kernels of a plan
into numba's on-disk cache while the parent goes on: for the continuation
(:meth:`~vibeam.models.core.shooting.ModalShooting.compile_corrector_ahead`) the tangent and the
corrector's callees that do not call the integrator at once, then, past a :data:`GATE` the
parent opens once it has compiled and cached the integrator (:func:`proceed`), the corrector.  The parent's shots then load the tangent instead of compiling
it, and :func:`wait` (before the corrector's first call) waits for the child and loads the
corrector.  On a 2-core machine the compilations overlap (issue 44's "compile independent entry
points in parallel processes into the shared on-disk cache"): a cold ``vibeam continue
cases/paper-fig13-continuation.toml --quick`` 63.9 -> 37.6 s (``vibeam bench --compile``'s probe).

The event integrator's first compile (any scene, the quick start's included) is helped the same
way through :func:`beside`: its callees (``_held_step``, ``_impact``, the scans, ...), whose
signatures a manifest recorded (:func:`callee_plan`), compile in a child from the last the
integrator reaches while the parent compiles from the first: quick start 19.8 -> 15.7 s of
compiling, Kelvin-Voigt point 37.9 -> 30.7 s (``vibeam bench --compile``).

What it does not change: the machine code (the child compiles the same signature with the same
numba configuration and the parent loads what it saved, as any later run would); the results.
If the child fails, is killed, or its cache entry cannot be loaded, the parent compiles the
kernel itself, as without this module.

It does nothing (the parent compiles everything, as before) unless all of these hold:

* the platform forks (``os.fork``, Linux: a forked child shares the parent's imported modules
  and compiles at once; elsewhere ``spawn`` would re-import everything);
* this process runs one thread (forking a multi-threaded process can deadlock the child) and may
  run on two cores or more (on one, the child would only take the parent's time);
* the kernel is neither compiled in this process nor in numba's cache (a warm run forks nothing);
* ``VIBEAM_COMPILE_AHEAD`` is not ``0``.

The child drops numba's event listeners it inherited (a progress line or a compile probe of the
parent's must not count its work as the parent's or as a pool worker's); the parent reports the
wait as compiling the kernel (one ``"numba:compile"`` event around the wait and the load), so the
time a user waits is still announced and measured as compiling.
"""
from __future__ import annotations

import contextlib
import importlib
import os
import pickle
import sys
import tempfile
import threading
from pathlib import Path

import numba
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
    pid = os.fork()
    if pid == 0:                                   # the child: compile, save, leave
        code = 1
        try:
            os.close(gate_w)
            code = _child(todo, gate_r)
        except BaseException:
            pass
        finally:
            os._exit(code)
    os.close(gate_r)
    record = {"pid": pid, "gate": gate_w if GATE in todo else None}
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


# ----------------------------------------------------------------------------- callees of an entry
# A kernel's callees (numba compiles them one after another inside the kernel's own compile) can
# be compiled by a child too, given their signatures: the child compiles them from the last one
# the kernel reaches while the parent compiles from the first; whatever the child has saved when
# the parent reaches it is loaded.  Their signatures are known only once the kernel has been
# compiled, so they are recorded then (numba types, pickled with numba's version) in a manifest:
# this machine's (beside numba's cache), else the one shipped with vibeam (recorded on the
# development machine by ``python -m vibeam.models.core.ahead``; numba's types do not depend on
# the machine).  A manifest of another numba is not used; a stale entry only costs the child time.

#: kernels whose callees are recorded and compiled ahead (:func:`beside`)
RECORDED: set = set()
#: the manifest shipped with vibeam
SHIPPED = Path(__file__).with_name("callees.pkl")


def local_manifest() -> Path:
    """This machine's manifest: beside numba's cache (``NUMBA_CACHE_DIR``), else in
    ``$XDG_CACHE_HOME/vibeam`` (``~/.cache/vibeam``)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "vibeam")
    return Path(base) / "vibeam-callees.pkl"


def _read_manifest(path) -> dict:
    """``{(module, qualname, signature): [(module, qualname, signature), ...]}`` of a manifest of
    this numba ({} if missing, unreadable or of another numba)."""
    try:
        with open(path, "rb") as f:
            d = pickle.load(f)
        return d["entries"] if d.get("numba") == numba.__version__ else {}
    except Exception:
        return {}


def _write_manifest(path, entries) -> None:
    """Write ``entries`` whole (a temporary file, fsync, rename: what
    :func:`vibeam.io.outdir.replace_file` does, which this layer cannot import); a file that cannot
    be written is skipped (it is only a head start)."""
    try:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".callees-", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                pickle.dump({"numba": numba.__version__, "entries": entries}, f)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except Exception:
        pass


def _name(dispatcher) -> tuple:
    return dispatcher.py_func.__module__, dispatcher.py_func.__qualname__


def _resolve(module: str, qualname: str):
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def callee_plan(dispatcher, sig) -> list | None:
    """The ``(dispatcher, signature)`` pairs of the callees recorded for ``dispatcher`` at ``sig``,
    from the last one compiled to the first (this machine's manifest, else the shipped one);
    None when neither has them."""
    key = _name(dispatcher) + (sig,)
    for path in (local_manifest(), SHIPPED):
        rows = _read_manifest(path).get(key)
        if rows:
            plan = []
            for module, qualname, csig in reversed(rows):
                try:
                    plan.append((_resolve(module, qualname), csig))
                except Exception:
                    continue
            return plan
    return None


class _Callees(event.Listener):
    """The callees compiled inside one outermost compilation, in the order they end."""

    def __init__(self):
        self.rows = []
        self.depth = 0

    def on_start(self, ev):
        self.depth += 1

    def on_end(self, ev):
        self.depth -= 1
        if self.depth >= 1:
            d = ev.data["dispatcher"]
            module, qualname = _name(d)
            if module.startswith("vibeam.") and "<locals>" not in qualname:     # not numba's own overloads
                self.rows.append((module, qualname, tuple(ev.data["args"])))


@contextlib.contextmanager
def beside(dispatcher, args):
    """Around the first call of a kernel of :data:`RECORDED` with ``args``: if it is to be compiled
    here and no child is at work already, a child compiles its recorded callees meanwhile
    (:func:`callee_plan`, :func:`start`; with two children at once, a continuation's first
    compile took longer: 38.6 s against 35.0);
    without a recorded plan, the callees this compile meets are recorded in this machine's
    manifest for the next one (after an edit of ``vibeam.models``, every kernel compiles again).
    Does nothing for other kernels, or when the kernel is compiled or cached."""
    _reap()
    if dispatcher not in RECORDED or _PENDING:     # a child has the second core already (a continuation's)
        yield
        return
    try:
        sig = _signature(args)
        if _load_cached(dispatcher, sig):
            yield
            return
        plan = callee_plan(dispatcher, sig)
    except Exception:
        yield
        return
    if plan:
        start([(d, s) for d, s in plan], signatures=True)
        yield
        return
    listener = _Callees()
    event.register("numba:compile", listener)
    try:
        yield
    finally:
        event.unregister("numba:compile", listener)
    if listener.rows and sig in dispatcher.overloads:
        path = local_manifest()
        entries = _read_manifest(path)
        entries[_name(dispatcher) + (sig,)] = listener.rows
        _write_manifest(path, entries)


def ship() -> Path:
    """Merge this machine's manifest into :data:`SHIPPED` (``NUMBA_CACHE_DIR=... python -m
    vibeam.models.core.ahead`` after a cold run of a scene on that empty cache: a kernel's entry
    is complete only when none of its callees was cached before; tests/README.md lists the runs)."""
    local = _read_manifest(local_manifest())
    if not local:
        raise SystemExit(f"no manifest of numba {numba.__version__} at {local_manifest()}: run a case cold first")
    entries = _read_manifest(SHIPPED)
    entries.update(local)
    _write_manifest(SHIPPED, entries)
    return SHIPPED


if __name__ == "__main__":      # pragma: no cover - a developer's step
    print(ship())
