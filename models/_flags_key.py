"""A cheaper hash and equality test of numba's compile flags, with the same results.

numba's typing templates cache the implementations of ``@overload`` and ``@njit`` callees
keyed on the argument types *and* the compile flags on top of numba's config stack
(``numba.core.typing.templates._OverloadFunctionTemplate._get_impl``).  Every lookup hashes the
flags and, on a hit with another flags object (every compilation makes its own), compares them:
``TargetConfig.__hash__`` is ``hash(tuple(sorted(self.values())))`` and ``__eq__`` compares
``self.values()``, each of which reads every one of the ~40 options through its property.
About 135,000 such calls take 0.9 s of the quick start's 23 s of compiling (measured with timers
around the two methods, 2026-11-26).

:func:`install` replaces them by the same functions computed faster:

* ``values()`` is a dict, so ``sorted`` of it sorts its *keys*: the hash is that of the sorted
  option names of the class, a constant per class, computed once;
* two flags objects of one class whose explicitly set options are equal have equal
  ``values()``; anything else is left to numba's own ``__eq__``.

The install is guarded: it checks, on flags objects it builds, that the new hash equals numba's
and that the fast equality agrees with numba's, and leaves numba alone otherwise (another numba
version may define them differently).  Idempotent; checked against numba 0.68.
"""
from __future__ import annotations


def install() -> bool:
    """Install the cheaper ``__hash__`` and ``__eq__`` of ``numba.core.targetconfig.TargetConfig``.

    Returns
    -------
    bool
        True when installed (now or before), False when numba's flags are not the ones this
        module was checked against (numba is then left as it is).
    """
    try:
        from numba.core import targetconfig
        from numba.core.compiler import Flags
    except ImportError:     # pragma: no cover - numba is a dependency
        return False
    base = targetconfig.TargetConfig
    if getattr(base, "vibeam_fast_key", False):
        return True
    numba_hash, numba_eq = base.__hash__, base.__eq__
    per_class: dict = {}

    def __hash__(self):
        cls = type(self)
        h = per_class.get(cls)
        if h is None:
            h = per_class[cls] = hash(tuple(sorted(cls.options)))
        return h

    def __eq__(self, other):
        if type(self) is type(other) and self._values == other._values:
            return True
        return numba_eq(self, other)

    # the guard: numba's own results on flags objects like the ones the compiler makes
    a, b, c = Flags(), Flags(), Flags()
    try:
        a.nrt = True
        b.nrt = True
        c.nrt = False
        c.boundscheck = True
        same = (numba_hash(a) == __hash__(a) == numba_hash(c) == __hash__(c)
                and numba_eq(a, b) is True and __eq__(a, b) is True
                and numba_eq(a, c) is False and __eq__(a, c) is False)
    except Exception:       # pragma: no cover - another numba
        same = False
    if not same:
        return False
    base.__hash__ = __hash__
    base.__eq__ = __eq__
    base.vibeam_fast_key = True
    return True
