"""numba's on-disk cache for the kernels of ``vibeam.models``, keyed on the whole package.

numba keys a cached kernel on its own source file only (a content hash of that
file and the bytecode of the decorated function).  The kernels here inline
functions of other modules of the package (``roots``, ``impact``,
``sdof_flow``, ``core.signals``): after one of those changes, numba would go on
loading the old machine code of every caller.  :func:`install` registers cache
locators, tried before numba's own, that serve every file of this folder and
whose source stamp is one hash of *all* ``*.py`` files of the folder
(:func:`package_stamp`): any change of any module invalidates every kernel of
the package, which is recompiled once and cached again.  Where the caches go
is numba's usual choice (``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the
sources, else the user-wide cache folder).

It also makes a damaged cache harmless: an index or data file that cannot be
read (zero length, truncated, garbage, from a killed write or a full disk) is
removed and the kernel is compiled afresh, instead of every call failing.

:func:`install` runs when ``vibeam.models`` is imported, before any kernel
module (``models/__init__.py`` imports this module first).  This module uses
numba internals (``numba.core.caching``), checked against numba 0.58-0.68.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

_DIR = Path(__file__).resolve().parent
_stamp: str | None = None


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


def _ours(py_file) -> bool:
    try:
        return _DIR in Path(py_file).resolve().parents
    except (OSError, TypeError, ValueError):
        return False


def install() -> None:
    """Register the package-wide cache locators and the damaged-cache guard (idempotent)."""
    from numba.core import caching

    if getattr(caching, "_vibeam_models_cache", False):
        return

    class _PackageStamp:
        """Mixin: serve only files of this folder; stamp = hash of the whole folder."""

        def get_source_stamp(self):
            return package_stamp()

        @classmethod
        def from_function(cls, py_func, py_file):
            if not _ours(py_file):
                return None
            return super().from_function(py_func, py_file)

    bases = [getattr(caching, n, None) for n in
             ("UserProvidedCacheLocator", "_UserProvidedCacheLocator",
              "InTreeCacheLocator", "_InTreeCacheLocator",
              "UserWideCacheLocator", "_UserWideCacheLocator")]
    seen, locators = set(), []
    for b in bases:
        if b is None or b in seen:
            continue
        seen.add(b)
        locators.append(type("VibeamModels" + b.__name__.lstrip("_"), (_PackageStamp, b), {}))
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")
    impl._locator_classes[:0] = locators
    ours = tuple(locators)

    original = caching.Cache.load_overload

    def load_overload(self, sig, target_context):
        if not isinstance(self._impl.locator, ours):
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
    caching._vibeam_models_cache = True
