"""One scope per copied callee while numba inlines a function: a compile-time fix, no change of code.

numba inlines a function declared ``inline="always"`` by copying its IR into the
caller (``numba.core.inline_closurecall.InlineWorker.inline_ir``).  The copy
deep-copies the callee's blocks one at a time, each with a fresh memo, and every
variable refers to the function's one scope, which holds every variable of the
function: so the whole scope is copied once per block, a cost of (blocks) x
(variables), quadratic in the size of the inlined function (numba issue #8989,
"Spurious deep copies in inlining", open; #9245 removed a part of it).  The
event loop's phases are inlined into :func:`vibeam.models.core.integrator.integrate_work`
and the shooting kernels, and the free step alone, with its own phases inlined,
is hundreds of blocks and thousands of variables.

:func:`install` makes the copies of one ``inline_ir`` call share one copy of the
scope: while ``inline_ir`` runs, ``numba.core.ir.Scope`` has a ``__deepcopy__``
that copies a scope the first time it is met and hands out that same copy to the
other blocks.  The copied IR is the one numba would build, except that its blocks
share one scope object instead of equal copies (numba's inliner already treats
them as one: it asserts a single scope, by equality, and afterwards points every
inlined block at the caller's scope).  The machine code is unchanged; the cache
key of a kernel does not depend on it.  It acts only when the inlined callee is a
function of ``vibeam.models``: another library's inlining in the same process is
numba's own.  Measured: :data:`GAINS_FROM`.

Used only where numba has the internals this was written against and where it
was measured to pay (:data:`GAINS_FROM`: numba 0.68 of the pinned range
0.61-0.68): ``InlineWorker.inline_ir`` exists and ``Scope`` defines no
``__deepcopy__`` of its own; otherwise :func:`install` leaves numba alone.
"""
from __future__ import annotations

import copy

import numba

#: the modules whose inlined callees get the shared scope: vibeam's kernels only
OURS = "vibeam.models"
#: the first numba release it is installed on: a cold quick start's process CPU, with and without,
#: alternately on one loaded 2-core machine (2026-11-26, two pairs each): numba 0.68.1 48.8 / 52.7 s
#: against 57.5 / 63.1 s (16 % less), numba 0.61.2 64.1 / 62.4 s against 67.8 / 64.7 s (5 %: below
#: the 10 % for which vibeam patches another library's internals, so numba is left alone there)
GAINS_FROM = (0, 68)


def install() -> bool:
    """Patch numba's inliner so that the blocks of one inlined copy share one scope (idempotent).

    Returns
    -------
    bool
        True if the patch is in place (now or before), False if this numba's internals differ
        from those it was written against (nothing is changed then).
    """
    try:
        from numba.core import inline_closurecall as icc, ir
    except ImportError:
        return False
    if tuple(int(x) for x in numba.__version__.split(".")[:2]) < GAINS_FROM:
        return False
    worker = getattr(icc, "InlineWorker", None)
    original = getattr(worker, "inline_ir", None)
    if original is None:
        return False
    if getattr(original, "vibeam_shared_scope", False):
        return True
    if "__deepcopy__" in vars(ir.Scope):
        return False
    state = {"depth": 0, "copies": {}}

    def scope_deepcopy(scope, memo):
        seen = state["copies"].get(id(scope))
        if seen is not None and seen[0] is scope:
            memo[id(scope)] = seen[1]
            return seen[1]
        new = object.__new__(type(scope))
        memo[id(scope)] = new
        state["copies"][id(scope)] = (scope, new)       # the original kept: its id is not reused
        new.__dict__.update(copy.deepcopy(scope.__dict__, memo))
        return new

    def inline_ir(self, caller_ir, block, i, callee_ir, *args, **kwargs):
        func = getattr(getattr(callee_ir, "func_id", None), "func", None)
        if not str(getattr(func, "__module__", "")).startswith(OURS):   # another library's inlining: numba's own
            return original(self, caller_ir, block, i, callee_ir, *args, **kwargs)
        if state["depth"] == 0:
            ir.Scope.__deepcopy__ = scope_deepcopy
        state["depth"] += 1
        try:
            return original(self, caller_ir, block, i, callee_ir, *args, **kwargs)
        finally:
            state["depth"] -= 1
            if state["depth"] == 0:
                del ir.Scope.__deepcopy__
                state["copies"].clear()

    inline_ir.vibeam_shared_scope = True
    inline_ir.__wrapped__ = original
    inline_ir.__doc__ = original.__doc__
    worker.inline_ir = inline_ir
    return True
