"""numba's on-disk cache for the kernels of ``vibeam.models``, keyed on the whole package.

numba keys a cached kernel on its own source file only (a content hash of that
file and the bytecode of the decorated function).  The kernels here inline
functions of other modules of the package (``core.roots``, ``impact``,
``core.oscillator``, ``core.signals``): after one of those changes, numba would go on
loading the old machine code of every caller.  :func:`install` registers cache
locators, tried before numba's own, that serve every file of this folder and
whose source stamp is one hash of *all* ``*.py`` files of the folder
(:func:`package_stamp`): any change of any module invalidates every kernel of
the package, which is recompiled once and cached again.  Where the caches go
is numba's usual choice (``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the
sources, else the user-wide cache folder).

It also makes two failures harmless:

* a damaged cache: an index or data file that cannot be read (zero length,
  truncated, garbage, from a killed write or a full disk) is removed and the
  kernel is compiled afresh, instead of every call failing;
* no writable cache anywhere (``NUMBA_CACHE_DIR`` unset or read-only, the
  sources' ``__pycache__`` and the user cache folder read-only): numba refuses
  to decorate a ``cache=True`` kernel ("no locator available", at import);
  here the kernels are cached in a temporary folder removed at exit, i.e. run
  uncached, with one warning line.

These use numba internals (``numba.core.caching``: the locator classes and
``CacheImpl._locator_classes``), checked against the pinned numba range
(``pyproject.toml``: 0.61-0.68, both ends tested by ``.ci/run``).  On a numba
whose internals differ, :func:`install` changes nothing and says so in one line:
vibeam then runs on numba's own cache (an edit of a callee module then needs
the cache cleared by hand).
"""
from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numba

_DIR = Path(__file__).resolve().parent
_stamp: str | None = None
_state: dict = {"installed": None, "temp": None}


def package_stamp() -> str:
    """SHA-256 over the names and contents of every ``*.py`` file of ``vibeam.models`` and its
    subpackages.

    Computed once per process (the sources of a running process do not change
    what it has already imported).

    Returns
    -------
    str
        Hex digest, e.g. ``'models-3f2a...'``.
    """
    global _stamp
    if _stamp is None:
        h = hashlib.sha256()
        for p in sorted(_DIR.rglob("*.py")):
            h.update(p.relative_to(_DIR).as_posix().encode() + b"\0")
            h.update(p.read_bytes() + b"\0")
        _stamp = "models-" + h.hexdigest()
    return _stamp


def ours(py_file) -> bool:
    """Whether ``py_file`` is a source file of this folder (``vibeam.models``)."""
    try:
        return _DIR in Path(py_file).resolve().parents
    except (OSError, TypeError, ValueError):
        return False


def _say(msg: str) -> None:
    try:
        sys.stderr.write(f"vibeam: warning: {msg}\n")
    except (OSError, ValueError):      # pragma: no cover - no stderr
        pass


def _internals():
    """``(caching, base locator classes, CacheImpl)`` of this numba, or raise ``AttributeError``
    naming the first internal that is missing."""
    from numba.core import caching

    names = ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
    bases = []
    for n in names:
        b = getattr(caching, n, None) or getattr(caching, "_" + n, None)
        if b is None:
            raise AttributeError(f"numba.core.caching.{n}")
        bases.append(b)
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None:
        raise AttributeError("numba.core.caching.CacheImpl")
    if not isinstance(getattr(impl, "_locator_classes", None), list):
        raise AttributeError("numba.core.caching.CacheImpl._locator_classes")
    if not callable(getattr(getattr(caching, "Cache", None), "load_overload", None)):
        raise AttributeError("numba.core.caching.Cache.load_overload")
    return caching, bases, impl


def install() -> bool:
    """Register the package-wide cache locators, the damaged-cache guard and the temporary
    fallback (idempotent).

    Returns
    -------
    bool
        True when installed (now or before); False when this numba's caching internals differ
        from those of the pinned range: nothing is changed then, and one warning line on stderr
        says that numba's own cache is used.
    """
    if _state["installed"] is not None:
        return _state["installed"]
    try:
        caching, bases, impl = _internals()
        _install(caching, bases, impl)
        _state["installed"] = True
    except Exception as exc:        # another numba: never fail the import of vibeam for a cache
        _say(f"numba {numba.__version__}'s cache internals differ from those vibeam was written for "
             f"(0.61-0.68; {type(exc).__name__}: {exc}); using numba's own cache: after editing a module "
             f"of vibeam.models, clear its cache (NUMBA_CACHE_DIR or models/__pycache__)")
        _state["installed"] = False
    return _state["installed"]


def _temp_root() -> str:
    if _state["temp"] is None:
        _state["temp"] = tempfile.mkdtemp(prefix="vibeam-numba-")
        atexit.register(shutil.rmtree, _state["temp"], True)
        _say(f"no writable numba cache (NUMBA_CACHE_DIR unset or read-only, {_DIR / '__pycache__'} and "
             f"the user cache folder read-only): kernels are compiled for this process only; set "
             f"NUMBA_CACHE_DIR to a writable folder to keep them")
    return _state["temp"]


def _install(caching, bases, impl) -> None:
    class PackageStamp:
        """Mixin: serve only files of this folder; stamp = hash of the whole folder."""

        def get_source_stamp(self):
            return package_stamp()

        @classmethod
        def from_function(cls, py_func, py_file):
            if not ours(py_file):
                return None
            return super().from_function(py_func, py_file)

    locators = [type("VibeamModels" + b.__name__.lstrip("_"), (PackageStamp, b), {}) for b in bases]

    user = bases[0]

    class VibeamModelsTemporaryLocator(PackageStamp, user):
        """The last resort for this folder's kernels: a temporary folder of this process."""

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(_temp_root(), self.get_suitable_cache_subpath(py_file))

        @classmethod
        def from_function(cls, py_func, py_file):
            if not ours(py_file):
                return None
            self = cls(py_func, py_file)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    impl._locator_classes[:0] = locators
    impl._locator_classes.append(VibeamModelsTemporaryLocator)
    mine = tuple(locators) + (VibeamModelsTemporaryLocator,)

    original = caching.Cache.load_overload

    def load_overload(self, sig, target_context):
        if not isinstance(getattr(getattr(self, "_impl", None), "locator", None), mine):
            return original(self, sig, target_context)
        try:
            return original(self, sig, target_context)
        except Exception:
            # unreadable index or data file: forget it; the kernel is compiled and saved afresh
            index = getattr(self._cache_file, "_index_path", None)
            if index:
                try:
                    os.unlink(index)
                except OSError:
                    pass
            return None

    caching.Cache.load_overload = load_overload
